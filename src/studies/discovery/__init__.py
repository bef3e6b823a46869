"""``studies discover``: what the simulation gets wrong, its cause, the extension, the gain."""
