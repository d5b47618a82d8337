"""DH-Robotics AG-95 / AG-105-145 over Modbus RTU: register map, link, driver."""
