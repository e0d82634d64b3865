"""The cameras of the videos: imported from a calibration or estimated (COLMAP's models in sfm, a
moving camera's frames registered in registration, the moving points' own cameras in
moving_points, one model's cameras or the moving points' instead in model_or_points), and which
set the joint vote trusts most (choice, over the sets of camera_set)."""
