"""The playback application: the player (ramp-in, streaming, safe stop), the drive (live velocity
commands from the keyboard, a gamepad or JSON lines, blended from a gait library; `drive`,
`command_sources`), the safety gate (limits, per-tick steps), pre-flight checks, the watchdog,
telemetry, calibration, fault specs for rehearsals, the thermal watch and the `gaitsmith-play run
| drive | calibrate | plot` commands (commands, drive_command). Every position it sends goes
through `hardware.bus`."""
