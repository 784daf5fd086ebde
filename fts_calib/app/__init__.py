"""App: the command line (argparse and dispatch), one module per command, text reports, plots and progress."""
