"""seawatch.io"""
