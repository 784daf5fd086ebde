"""Sources: where samples come from, as one record (SampleBatch).

Recordings and recording sets, ROS 2 bags, UDP datagrams, a UR arm; the synchronizer, the writer and the sender.
Knows nothing of kinematics, filters or the estimator.
"""
