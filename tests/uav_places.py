"""Where the UAV tests fly: the base of the shipped scenarios (lat, lon, alt) and points given in metres east and
north of it, written as a scenario YAML's ``[lat, lon]``."""
from uavsim.geodesy import geodetic_from_enu

BASE = (-7.275, -35.965, 540.0)


def latlon(east: float, north: float, digits: int = 8) -> list[float]:
    lat, lon, _ = geodetic_from_enu(east, north, 0.0, *BASE)
    return [round(float(lat), digits), round(float(lon), digits)]
