"""The warehouse patrol: a second task for ReFrESH, larger than the paper's.

Three robots (rover1 patrolling a painted line, rover2 docked with a free CPU, a fixed mast with
an overhead camera), thirteen modules in six schemas with alternatives on all three, two of them
guest modules in C that migrate. It is an application of the framework (`application`): this
package declares it, and the framework makes its command, its runs in process and across
processes, its reports and campaigns.

================  ==========================================================================
``declaration``   `APPLICATION`: the database, scenarios, natives, guests, what a run samples
                  (rover1's pose against the line) and draws
``track``         the patrol line: a stadium, and a pose's offset and heading error against it
``firmware``      the native E-PBOs: sensors, the median filter, the PID, the drives, the chassis
``guest/``        the guest E-PBOs in C: Kalman (filter) and Pursuit (controller)
``patrol.toml``   the module database and the task
``scenarios``     the faults of each scenario, set as the modules' fault_at constants
``campaign``      the faults a campaign draws
================  ==========================================================================
"""
