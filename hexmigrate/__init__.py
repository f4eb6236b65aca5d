"""hexmigrate: ReFrESH modules as extended Intel HEX, and their migration between nodes.

`hexmigrate.records` is the codec (records 00-05 plus 07 and 08), `hexmigrate.image` the
relocatable `ModuleImage`, `hexmigrate.elf` and `hexmigrate.mapfile` build images from linker
output, and `hexmigrate.cli` is the `hexmigrate` command.
"""
