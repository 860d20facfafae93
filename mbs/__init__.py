"""Baukasten"""
