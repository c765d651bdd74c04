"""The contact between peg and hole: the model of eq. 5-13, the features, the segmentation into
states and the boundary mapping."""
