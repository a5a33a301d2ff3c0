"""seawatch.camera"""
