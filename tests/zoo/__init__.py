"""The zoo: robot folders that are not built-ins (see tests/zoo/fixtures.py)."""
