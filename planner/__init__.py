"""Spacetime gait planner (W&P 2009 §3-4), gait templates and basin-CMA."""
