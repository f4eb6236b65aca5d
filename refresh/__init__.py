"""refresh: ReFrESH decision making and system maintenance (the paper's sections 3.2, 4 and 6).

One concept per module or subpackage:

===================  =======================================================================
``errors``           the exception tree under RefreshError
``database``         the module database tree: robots, schemas, modules, placements
``schema``           the JSON Schema of a database file and its error wording
``task``             the task specification T: state machine, schemas, metrics, alpha
``load``             reading a TOML database (and task) file with full validation
``images``           the module images a database names, checked against its modules
``configuration``    a configuration C: chains per slot, robots, port connections
``performance``      equations (1)-(5): P_NF, P_F, P_T, Util, the best configuration
``estimators/``      what a configuration that does not run would achieve: the Estimator, its
                     back ends (a function, pbort shadow runs) and the host's factory
``decider``          phase 1: evaluator buffers -> violation, with debounce
``location/``        phase 2: fault location, Base Choice and three other strategies
``generator``        phase 3: alternatives, combo modules, placements, greedy choice
``adaptation``       the three phases in a row: one decision
``maintainer``       the plan from one configuration to another, applied step by step
``appliers/``        the plan carried out: one base, and its back ends in memory, on nodes in
                     this process and on nodes over links
``remote/``          the manager's side of a node over a link: requests, pushed reports
``events``           the event log of every decision, on a clock of the caller's
``cli``              ``python -m refresh``: check, cases, manage
``runtime/``         the run loop for any task: deploy, watch, decide, repair
``manager/``         ``python -m refresh manage``: the runtime over the links to a task's nodes
``synthetic``        random databases and estimators, for benchmarks and property tests
===================  =======================================================================
"""
