"""The visual-servoing task of the paper's section 6 as E-PBOs (executor, evaluator, estimator).

`camera` reads frames from a camera device (CamReader, CamReader_alt), `matcher` finds the
current target by template matching (SSD, SSD_alt), `trajectory` cycles through the targets and
turns the platform towards them (TrajGen, TrajGen_alt); HexMan is `hexmanipulator.hexman_pbo`,
the Dehazer is guest code (`visual_servoing.dehazer_guest`). Every module's evaluator reports its
power (non-functional 0, in the module database's normalized units), and SSD's the paper's
functional metric: the horizontal deviation of the target from the image centre.
"""
