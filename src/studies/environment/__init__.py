"""Environment acting on the ship: wind loads, current, disturbances, sensor noise."""
