"""Writing rtval's HTML pages: one template environment and the pages' security policy."""
