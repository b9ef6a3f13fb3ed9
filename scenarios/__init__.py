"""Scenario files shipped with nanoblock, importable as package data ``nanoblock.scenarios``."""
