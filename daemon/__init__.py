"""cyborgd: the rig's device daemon, offline analysis tools and the science core."""
