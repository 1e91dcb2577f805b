"""The survey: the station's state machine and what it leans on (where the rig stood, what
earlier stations saw, registration to them, the session's report)."""
