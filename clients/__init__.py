"""Clients of the rig's bus: a library (:mod:`clients.rigclient`), the demo, the CLI."""
