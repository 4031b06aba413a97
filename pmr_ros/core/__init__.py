"""The numerical core: models, plant, PRBS, MPC, spectra and both PMR methods; numpy/scipy only, never rclpy."""
