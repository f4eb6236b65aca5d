"""The module transfer protocol: messages in two modes, the node's receiver, the sender."""
