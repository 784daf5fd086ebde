"""Export a calibration for firmware (a C header) and for ROS 2 (ros2_control parameters).

A microcontroller computes the wrench itself from the C header's ``FTS_CALIB_C`` and
``FTS_CALIB_D`` (float, or double with ``FTS_CALIB_DOUBLE``); a ROS 2 robot gets the
``force_torque_sensor_broadcaster`` offsets and a ``GravityCompensationWrench`` filter for
its payload. The example writes both, reads the header's numbers back and evaluates the
header's loop in Python beside ``WrenchReader`` on the same sample.
"""

import re
import tempfile
from pathlib import Path

import numpy as np

import fts_calib

NUMBER = r"[-+]?\d+(?:\.\d+)?(?:e[-+]?\d+)?"


def main():
    """Write the two exports, then check the header against the reader and print the ROS 2 payload."""
    sensor = fts_calib.load_simulated_sensor("sensor")
    calibration = fts_calib.load_calibration("paper_table1_calibration")  # Table 1 of the paper
    calibration = calibration.with_offsets(sensor.D, "re-tare (here: the simulated sensor's offsets)")
    gripper = fts_calib.load_tool("validation_tool").configurations[0]  # the payload the filter removes
    with tempfile.TemporaryDirectory() as folder:
        header = Path(folder) / "fts_calib.h"
        header.write_text(fts_calib.export(calibration, "c-header"))
        params = Path(folder) / "ft_sensor.yaml"
        params.write_text(fts_calib.export(calibration, "ros2", payload=gripper))
        text = header.read_text()
        lines = len(params.read_text().splitlines())
        print(f"wrote {header.name} ({len(text.splitlines())} lines) and {params.name} ({lines} lines), in a temporary folder")
        ros2 = params.read_text()
    # the header's numbers, read back as a C compiler would (FTS_CALIB_R(x) is x)
    C = np.array([float(v) for v in re.findall(rf"FTS_CALIB_R\(({NUMBER})\)", text.split("FTS_CALIB_D[6]")[0])]).reshape(6, 8)
    D = np.array([float(v) for v in re.findall(rf"FTS_CALIB_R\(({NUMBER})\)", text.split("FTS_CALIB_D[6]")[1])])
    channels = sensor.channels(np.array([5.0, -3.0, 12.0, 0.4, -0.2, 0.1]))  # [mV/V] under a known load
    in_header = np.array([D[i] + sum(C[i, k] * channels[k] for k in range(8)) for i in range(6)])  # the header's loop
    reader = fts_calib.WrenchReader(calibration).wrench(channels)
    print("header loop:  ", " ".join(f"{v:+.6f}" for v in in_header), "[N, N·m]")
    print("WrenchReader: ", " ".join(f"{v:+.6f}" for v in reader), "[N, N·m] (expected: the same)")
    print("applied load: ", " ".join(f"{v:+.6f}" for v in [5.0, -3.0, 12.0, 0.4, -0.2, 0.1]), "[N, N·m] (Table 1's rounding apart)")
    tool = re.search(r"CoG: \[(.*)\]\n\s+mass: (.*)\n\s+gravity_field: \[(.*)\]", ros2)
    print(f"ROS 2 gravity compensation: mass {tool.group(2)} kg, CoG [{tool.group(1)}] m in ft_sensor, gravity [{tool.group(3)}] m/s²")
    print(f"expected: mass {gripper.mass} kg, CoG {gripper.p_sensor_com.tolist()} m (the validation tool's configuration V)")


if __name__ == "__main__":
    main()
