"""gaitsmith's domain package: robots, servos, contact schedules and the gait file."""

from robots.errors import GaitFileError, RobotConfigError, RobotsError
from robots.robot import Joint, Leg, Robot, builtin_names, load
from robots.servo import ServoModel, load_catalogue, servo_model

__all__ = [
    "GaitFileError",
    "Joint",
    "Leg",
    "Robot",
    "RobotConfigError",
    "RobotsError",
    "ServoModel",
    "builtin_names",
    "load",
    "load_catalogue",
    "servo_model",
]

from robots.gait import SCHEMA, Gait, Velocity
from robots.schedule import ContactSchedule, ScheduleError

__all__ += ["SCHEMA", "ContactSchedule", "Gait", "ScheduleError", "Velocity"]
