"""Cross-view track pairs: by keyframe descriptors (descriptors), by epipolar votes over candidate
offsets (votes), the joint vote on every camera's offset with the rules that accept its choices
(joint), and point transfer into a third camera (transfer)."""
