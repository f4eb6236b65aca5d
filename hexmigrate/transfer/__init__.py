"""The module transfer protocol: its messages, each declared once (`messages`, with how each field
travels in `fields` and the generic codec in `layout`), the node's `receiver` and the `sender`."""
