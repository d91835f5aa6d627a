"""Volume data (CT, MRI, segmentations): the grid in physical space, its orientation on the
display, and what povh3d makes of it (surfaces, participating media)."""
