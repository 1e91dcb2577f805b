"""The pointing model: the camera's pinhole model, pixels <-> pan/tilt, and the mosaic's
geometry. The one home of the pixel-centre rule; the PTU and camera packages both use it."""
