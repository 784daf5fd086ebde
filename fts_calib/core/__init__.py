"""Core: exceptions, array and value checks, bounded parsing, files and shipped data.

Files: atomic writes, the one output guard, output paths. Knows nothing of the rest of the package.
"""
