"""`gaitsmith robots init`: scaffold a robot folder from a URDF or MJCF (`robots.scaffold.init`)."""

from robots.scaffold.errors import ScaffoldError
from robots.scaffold.init import InitResult, Questions, init_robot

__all__ = ["InitResult", "Questions", "ScaffoldError", "init_robot"]
