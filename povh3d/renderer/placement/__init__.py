"""Where the display sits in the scene, and which rays a method may start where."""
