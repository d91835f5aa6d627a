"""A model or a volume placed on povh3d's own stage (the scene povh3d writes around it)."""
