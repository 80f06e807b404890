"""The basics every layer uses: the version and code fingerprint, the error classes, the paper's
numbers, argument checks, files (atomic writes, npz with metadata, output locks), checkpoints,
progress bars, the parallel runner and pose algebra.
"""
