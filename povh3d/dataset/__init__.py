"""Exports of rendered light fields in the layouts research tools load."""
