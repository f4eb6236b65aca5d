"""refresh: ReFrESH decision making and system maintenance (the paper's sections 3.2, 4 and 6).

One concept per module:

======================  ======================================================================
``errors``              the exception tree under RefreshError
``database``            the module database tree: robots, schemas, modules, placements
``schema``              the JSON Schema of a database file and its error wording
``task``                the task specification T: state machine, schemas, metrics, alpha
``load``                reading a TOML database (and task) file with full validation
``images``              the module images a database names, checked against its modules
``configuration``       a configuration C: chains per slot, robots, port connections
``performance``         equations (1)-(5): P_NF, P_F, P_T, Util, the best configuration
``estimator``           the Estimator protocol and its plain-function back end
``kernel_estimator``    the Estimator back end on pbort shadow runs
``decider``             phase 1: evaluator buffers -> violation, with debounce
``location``            phase 2: fault location, Base Choice and three other strategies
``generator``           phase 3: alternatives, combo modules, placements, greedy choice
``adaptation``          the three phases in a row: one decision
``maintainer``          the plan from one configuration to another, applied step by step
``memory_applier``      an in-memory applier: the plan's effect on a model of the robots
``node_applier``        the applier on emulated nodes (firmware_sim) with hexmigrate transfers
``events``              the event log of every decision, on a clock of the caller's
``runtime``             the run loop for any task: deploy, watch, decide, repair (a package)
``remote.reports``      a robot's performance buffers filled from its node's pushed reports
``remote.remote_node``  one node over its link: requests and pushes on one reader
``remote.applier``      the applier over links (nodes in other processes), with bridges
======================  ======================================================================
"""
