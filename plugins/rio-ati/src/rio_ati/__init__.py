"""rio-ati: ATI Industrial Automation force/torque sensors for RIO (the Net F/T box over RDT), with an
emulator of the box. The driver is `rio_ati.driver.NetFTSensor` (`ati.netft`); the protocol `rio_ati.rdt`,
the calibration `rio_ati.calibration`, the emulator `rio_ati.emulator.NetFTBox`."""
