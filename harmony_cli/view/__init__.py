"""Replays of run directories in the browser (viser): `harmony view`."""
