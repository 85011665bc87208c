"""Judging an image against a target model, and `rtval compare` of two images."""
