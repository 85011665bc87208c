"""The diagnosis: which changes to a demo model explain an image, and the evidence for them."""
