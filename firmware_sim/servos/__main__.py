"""``python -m firmware_sim.servos``: see firmware_sim.servos.cli."""

from firmware_sim.servos.cli import main

raise SystemExit(main())
