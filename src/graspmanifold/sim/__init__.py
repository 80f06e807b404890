"""The simulated world: the Shadow Hand's MJCF and its joints and segments, the objects (primitives,
meshes, the object family), postures, tactile sensing, the MuJoCo scene, pictures, and many scenes
stepped together (on the CPU or with MuJoCo Warp).
"""
