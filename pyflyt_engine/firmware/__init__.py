"""Flight controller firmware in the loop: Betaflight's SITL target as a vehicle's controller (docs/firmware.md)."""
