"""The ICP DAS M8194H back end (ET-M8194H over Modbus TCP, RS-M8194H over Modbus RTU)."""
