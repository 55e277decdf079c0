"""Methods: whole methods built from reusable steps.

:mod:`suspenv.methods.tey2014` reproduces the parameter-identification method of Tey et
al. (2014) step by step. Curve identification fits the axle to whole K&C curves
(:mod:`~suspenv.methods.identify`, :mod:`~suspenv.methods.curve_fit`,
:mod:`~suspenv.methods.identifiability`).
"""
