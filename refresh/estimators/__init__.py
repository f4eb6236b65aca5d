"""refresh.estimators: what a configuration that is not running would achieve (E-PBO ES).

============  ==================================================================================
``base``      `Estimator`, its `Values`, and the `EstimatorFactory` the runtime asks at each
              decision
``function``  `FunctionEstimator`: a plain function of the configuration (tests, benchmarks)
``kernel``    `KernelEstimator`: the modules' estimators wired in a pbort shadow run
``host``      `HostEstimators`: kernel estimators on the manager's host node, which holds every
              module's code (`host_codes`, `host_estimators`)
============  ==================================================================================
"""
