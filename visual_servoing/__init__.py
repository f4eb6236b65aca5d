"""The visual-servoing task's building blocks: a camera scene, camera faults, SSD matching and the
Dehazer (a guest RV32 module in C with its numpy reference). docs/visual-servoing.md describes
them; the task's E-PBOs and the experiment (docs/experiment.md) build on them.

One concept per module:

==================  =========================================================================
``errors``          the exception tree under ServoingError
``frames``          check_frame: what a grey frame is (2-D uint8)
``shapes``          the targets' sprites: circle, square, triangle
``scene``           Scene: targets around the platform, render(yaw), templates, ground truth
``image_faults``    Gaussian and salt-and-pepper noise, fog, blackout; FaultSchedule
``ssd``             match_template: the SSD reference (OpenCV TM_SQDIFF)
``dehaze``          the Dehazer's algorithm in numpy: the guest's byte-exact reference
``dehazer_guest``   build the guest Dehazer (guest/dehazer.c) into a module image
``frame_player``    FramePlayer: a native PBO that plays frames into a kernel
``figure``          ``python -m visual_servoing.figure OUT.png``: the docs' frames figure
``task``            the task's E-PBOs: cameras, SSD matchers, trajectory generators
``experiment``      the two-robot world, the scenarios, the run and its report;
                    ``python -m visual_servoing run`` (docs/experiment.md)
==================  =========================================================================
"""
