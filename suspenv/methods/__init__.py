"""Methods: whole methods built from reusable steps, one package each.

:mod:`suspenv.methods.tey2014` reproduces the parameter-identification method of Tey et
al. (2014) step by step; :mod:`suspenv.methods.curves` (curve identification) fits the
axle to whole K&C curves. Neither imports the other: ``suspenv identify --method
tey2014`` reaches the paper's pipeline through the registry.
"""
