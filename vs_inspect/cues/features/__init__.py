"""Local features and their matching: learned features with the weights their packages ship
(learned), nearest-neighbour matching (nearest_neighbours) and matching guided by two-view
geometry (guided)."""
