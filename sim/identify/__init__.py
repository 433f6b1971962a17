"""Servo identification (issue #18 item 6): fit each servo's position gain, goal latency and
strength from an excitation run recorded with the robot lifted (`gaitsmith-play identify`).

`lifted_joint`: the one-joint model the fit simulates (the servo law of `sim.servo` on the
joint's inertia and gravity from the MJCF); `fit`: the record, the least-squares fit and its
check on held-back data; `plot`: the fit against the record.
"""
