"""CMM calibration from ball-plate measurements: kinematic and Gaussian-process error models."""
