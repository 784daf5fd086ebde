"""Core: exceptions, array and value checks, atomic file writing, YAML loading and shipped-data lookup.

Knows nothing of the other stages; every other stage may import it.
"""
