"""The playback application: the player (ramp-in, streaming, safe stop), the safety gate
(limits, per-tick steps), pre-flight checks, the watchdog, telemetry, calibration, fault specs
for rehearsals, the thermal watch and the `gaitsmith-play run | calibrate | plot` commands
(commands). Every position it sends goes through `hardware.bus`."""
