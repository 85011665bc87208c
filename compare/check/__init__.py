"""`rtval check`: the regression check of a renderer against baselines or a target model."""
