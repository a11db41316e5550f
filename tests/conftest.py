"""Shared test configuration.

Its presence puts ``tests/`` on ``sys.path`` (pytest's rootdir-relative import), so every test
module can ``from strategies import robots``.
"""
