"""What a render writes besides its image: views, depth maps, datasets, quilts, masks."""
