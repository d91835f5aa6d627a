"""The display: what the panel and its lens sheet are (presets, mappings, devices, sheets)."""
