"""cyborgd: the rig's device daemon, offline analysis tools and the science core."""

import importlib.metadata

__version__ = importlib.metadata.version("cyborg-astrobiologist")
