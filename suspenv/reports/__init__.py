"""Reports: Markdown, JSON and PNG figures of runs, problems, methods and diagnoses.

The only package that imports matplotlib; :func:`suspenv.reports._mpl.pyplot` selects the
non-interactive Agg backend once, on the first figure (importing a report module does not
import matplotlib). Reports sit above every library layer (they read problems, runs,
methods and diagnoses); those layers reach a report only through the names registered
in :mod:`suspenv.registry` (``report_function``), resolved when first called.

Modules: :mod:`.run` (convergence, Pareto), :mod:`.analysis` (runs compared),
:mod:`.kc_identification`, :mod:`.knc_rig` (K&C rig curves), :mod:`.minibus`,
:mod:`.minibus_ride`, :mod:`.suspension`, :mod:`.planar`, :mod:`.tey2014`,
:mod:`.diagnosis` (component, K&C, ride, road); cells and tables come from
:mod:`suspenv.core.markdown`, plain JSON values from :mod:`suspenv.core.jsonable`.
"""
