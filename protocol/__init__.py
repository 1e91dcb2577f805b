"""The rig's wire contract: key expressions, the msgpack envelope and its messages.

Pure: no zenoh, no asyncio, no hardware. Clients depend on this package only.
"""
