"""The benchmark suite: named, versioned instances with a known optimum, a target or a
reference front (:mod:`suspenv.suite.instances`), the shipped reference fronts
(:mod:`suspenv.suite.fronts`), and strategies run over it (:mod:`suspenv.suite.runner`)."""
