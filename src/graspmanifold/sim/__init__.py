"""The simulated world: the Shadow Hand's MJCF and its joints and segments (and the community's hand
models behind the same interface), the objects (primitives, meshes, the object family), postures, tactile
sensing, the MuJoCo scene, pictures, and many scenes stepped together (on the CPU or with MuJoCo Warp).
"""
