"""POV-Ray runs before or beside the render: the scene camera, the depth pass, object masks."""
