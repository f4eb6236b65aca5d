"""The module SDK: the C ABI header, the linker script and example modules for RV32IM guests.

`module_sdk.build` compiles a module's C file into the ELF, map, raw binary and plain
Intel HEX from which `hexmigrate` makes an extended HEX module image.
"""
