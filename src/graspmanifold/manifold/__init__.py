"""The grasp manifold: the Self-Organising Map and its compiled kernels, masked nearest search,
posture sets, the experience bases the controller recalls from, and the analyses and plots of maps.
"""
