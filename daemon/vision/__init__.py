"""The science core: pure numpy/OpenCV functions, arrays in, new arrays out."""
