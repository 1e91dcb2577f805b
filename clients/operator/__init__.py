"""``cyborg operator``: the remote operator's web console (aiohttp, no front-end build)."""
