"""refresh.appliers: the Maintainer's plan carried out on the robots, one base and its back ends.

=============  =================================================================================
``base``       `Applier` (the steps a plan needs) and `ApplierBase`, what every applier does:
               robots lost and rejoined, sources and reads, images and migrations, bridges
               between robots put up and taken down
``in_memory``  `MemoryApplier`: a model of the robots, the fake back end for tests of plans
``in_process`` `NodeApplier`: emulated nodes in this process (firmware_sim), migrations over
               an in-process link or a modelled wire in virtual time
``over_links`` `LinkApplier`: nodes in other processes or on boards, reached by URL
               (`refresh.remote`)
=============  =================================================================================
"""
