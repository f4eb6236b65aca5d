"""firmware_sim.cli: the ``firmware-sim`` command (``python -m firmware_sim``).

==============  ===========================================================================
``command``     the parser and the subcommands: run, listen, transfer, info
``arguments``   its argument types, each with its range
``run_report``  what ``firmware-sim run`` reports, as text and as JSON
==============  ===========================================================================
"""
