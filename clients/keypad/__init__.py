"""``cyborg keypad``: the field scientist's full-screen client for a small keyboard and a
head-mounted display (80×24, no mouse)."""
