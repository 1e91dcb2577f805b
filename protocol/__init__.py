"""The rig's wire contract: key expressions, the msgpack envelope and its messages.

Pure: no zenoh, no asyncio, no hardware; except :mod:`.link`, the one module that imports
zenoh and asyncio (it opens sessions and hands zenoh's callbacks to the event loop).
Clients depend on this package only.
"""
