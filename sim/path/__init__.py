"""Path following in MuJoCo (`gaitsmith drive-sim`): path specs and their arc-length
parametrisation (`spec`), the pure-pursuit controller on the measured base pose (`pursuit`),
the closed-loop rollout through the gait blender (`follow`), its metrics (`metrics`), and the
drawing of the path and footprints (`draw`)."""
