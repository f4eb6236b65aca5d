"""hexmigrate: ReFrESH modules as extended Intel HEX, and their migration between nodes.

`records` is the codec (records 00-05 plus 07 and 08, with its vectorised fast path in `bulk`
and its exception tree in `errors`); `image` holds the relocatable `ModuleImage`; `elf` and
`mapfile` build images from linker output; `descriptor` reads the PBO module descriptor;
`report` and `cli` make the `hexmigrate` command.
"""
