"""The render pipeline: request -> placement -> passes -> methods -> shots -> outputs."""
