"""seawatch.sim"""
