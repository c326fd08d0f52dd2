"""Reading and writing: images, videos and particle caches."""
