"""The link between the I/O process and the control process: messages, codec, the status record."""
