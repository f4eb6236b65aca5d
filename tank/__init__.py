"""The tank: the tutorial's task (docs/tutorial.md) as an application of the framework.

A water tank on two robots: robot a's level gauge feeds the level alarm, a guest module in C that
opens the inlet valve below its band; robot b has a backup gauge. The files are the tutorial's:

==================  ==========================================================================
``tank.toml``       the module database and the task
``tank_natives``    the native E-PBOs: the gauges
``level_alarm.c``   the guest E-PBO: the level alarm
``declaration``     `APPLICATION`: the scenarios, what a run samples, what a campaign draws
``tank_qemu.toml``  the same task with robot b on the C firmware (QEMU): docs/firmware.md
``backup_gauge.c``  robot b's backup gauge as a guest module, for that node
==================  ==========================================================================
"""
