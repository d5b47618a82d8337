"""Robotiq 2F-85 / 2F-140 / Hand-E: register map, the Modbus RTU and URCap links, the driver."""
