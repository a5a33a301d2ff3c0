"""seawatch.track"""
