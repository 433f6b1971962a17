"""gaitsmith command-line wiring: `gaitsmith` (plan / simulate / robots)."""
