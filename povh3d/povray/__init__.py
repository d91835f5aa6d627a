"""povray"""
