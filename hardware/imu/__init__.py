"""IMU drivers for the player's attitude feedback (`hardware.play.attitude.AttitudeSource`).

Device drivers live beside the servo bus drivers (`hardware.bus`), not in the player: the
player only knows the `AttitudeSource` protocol; `witmotion` is the WitMotion serial family.
"""
