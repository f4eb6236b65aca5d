"""refresh.manager: ReFrESH managing a task whose robots' nodes run in other processes.

``python -m refresh manage`` is made of these pieces, each usable on its own (an application
that runs its own robots across processes builds the same manager from them):

================  ===========================================================================
``time_modes``    the two time modes: `LockStep` (a `TimeMaster` grants the nodes quanta) and
                  `RealTime` (the host's monotonic clock); each checks the nodes run in it
``plant``         `Plant`: the caller's model of the world around the task, consulted each
                  look (live inputs of the estimators, samples, its own events), and `View`
``session``       `Session`: the one loop of a managed run, on any applier and time mode
``event_stream``  `EventStream`: each event printed and written as a JSON line as it comes
``manager``       `ManagerConfig` and `manage`: open the nodes, deploy, decide and repair;
                  `load_task`, `check_nodes` and `load_plant`: what the command is given,
                  checked before anything is deployed
================  ===========================================================================
"""
