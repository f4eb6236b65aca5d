"""The emulated node package; the module SDK lives in `firmware_sim.sdk`."""
