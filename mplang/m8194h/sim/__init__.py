"""The virtual M8194H: controller memory, macro interpreter and motion model."""
