"""The cameras of the videos: imported from a calibration or estimated (COLMAP's models in sfm, a
moving camera's frames registered in registration, the moving points' own cameras in
moving_points), and which set the joint vote trusts most (choice)."""
