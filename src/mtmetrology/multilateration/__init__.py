"""Sequential multilateration: machine errors from tracking-interferometer lengths."""
