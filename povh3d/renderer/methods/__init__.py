"""The rendering methods, their registry and the quality model."""
