"""The judge: pure functions of images and scenes. It reads and writes image files but never
starts a process or writes a page. `evaluate.evaluate_pair` is the one evaluation of a pair."""
