"""What the tests and the benchmarks share: rigs, waits, ports, ground stations, missions.

Plain modules, importable without pytest (the benchmarks run in a plain install); the pytest
fixtures built on them live in ``tests/conftest.py``.
"""
