"""The CAN link's defaults, apart from the link itself so that code that only reasons about a CAN
bus (the node's wire simulation times ISO-TP frames in virtual time) needs no python-can."""

HOST_IDS = (0x7E0, 0x7E8)
"""A host sends on 0x7E0 and listens on 0x7E8; a node the reverse (OBD-II's diagnostic pair)."""
DEFAULT_BITRATE = 500_000
"""bit/s of a bus whose URL names none."""
DEFAULT_PADDING = 0xCC
"""The byte that fills every frame to 8 bytes unless the URL says padding=off."""
