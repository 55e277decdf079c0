"""The K&C family: McPherson axle rig loops (:mod:`~suspenv.diagnosis.knc.family`)."""
