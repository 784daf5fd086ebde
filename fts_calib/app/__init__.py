"""App: the command line: options declared once, the parser, exit codes and one module per command."""
