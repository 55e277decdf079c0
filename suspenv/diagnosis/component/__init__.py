"""The component family: one component (damper, MR damper, friction guide, quarter car on a rig)."""
